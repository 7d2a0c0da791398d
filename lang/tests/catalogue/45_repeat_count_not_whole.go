// RepeatFor needs a whole number of repetitions, 0 or more.
package BadCount

var D1 Quadcopter

func INIT() {
	RepeatFor(-1, SEQ_Lap)
	RepeatFor(2.5, SEQ_Lap)
	RepeatFor(D1.Battery(), SEQ_Lap)
}

func SEQ_Lap() {
	D1.FlyByX(1)
}
