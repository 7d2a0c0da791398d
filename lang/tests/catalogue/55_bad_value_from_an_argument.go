// Values that are wrong only once a call supplies them: the error points at
// the use and at the call.
package ValueFromCall

var D1 Quadcopter

func INIT() {
	SEQ_Laps(3)
	SEQ_Laps(-2)
	SEQ_Scaled(0)
}

func SEQ_Laps(n int) {
	RepeatFor(n, SEQ_Lap)
}

func SEQ_Scaled(k float64) {
	D1.FlyByX(10 / k)
}

func SEQ_Lap() {
	D1.FlyByX(1)
}
