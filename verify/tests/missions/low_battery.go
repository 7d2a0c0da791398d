// A battery cannot be above 120 percent: the photo never happens.
package Low

var D1 Quadcopter

func SEQ_Main() {
	D1.Arm()
	If(D1.Battery() > 120, SEQ_Photo)
	D1.Disarm()
}

func SEQ_Photo() {
	D1.TakePhoto()
}
