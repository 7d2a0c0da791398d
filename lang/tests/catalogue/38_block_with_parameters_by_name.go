// A block with parameters cannot be passed by name, with or without
// parentheses.
package ParamsByName

var Drone1 Quadcopter

func INIT() {
	RepeatFor(3, SEQ_Square)
	RepeatFor(2, SEQ_Square(Drone1, 1))
}

func SEQ_Square(d Quadcopter, side float64) {
	d.FlyByX(side)
	d.FlyByY(side)
	d.FlyByX(-side)
	d.FlyByY(-side)
}
